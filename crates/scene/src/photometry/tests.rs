//! The parsers against hand-written files: symmetries folded the way the
//! formats define them, IES and EULUMDAT of one distribution giving one
//! table, exact flux of a closed-form distribution, and bad files refused
//! by file:line:field without a panic.

use super::*;

/// An asymmetric test distribution, cd: different in every quadrant.
fn f(g: f64, c: f64) -> f64 {
    let (g, c) = (g.to_radians(), c.to_radians());
    (100.0 + 40.0 * c.cos() + 15.0 * (2.0 * c).sin() + 7.0 * c.sin()) * (1.0 + g.cos())
}

/// `f` made symmetric the way `sym` says (so a reduced file is exact).
fn f_sym(sym: Symmetry, g: f64, c: f64) -> f64 {
    match sym {
        Symmetry::Rotational => f(g, 0.0),
        Symmetry::Full => f(g, c),
        Symmetry::BilateralC0 => 0.5 * (f(g, c) + f(g, 360.0 - c)),
        Symmetry::BilateralC90 => 0.5 * (f(g, c) + f(g, 180.0 - c)),
        Symmetry::Quadrant => {
            0.25 * (f(g, c) + f(g, 360.0 - c) + f(g, 180.0 - c) + f(g, 180.0 + c))
        }
    }
}

fn join(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

const GAMMAS: [f64; 7] = [0.0, 15.0, 30.0, 60.0, 90.0, 135.0, 180.0];

fn planes(sym: Symmetry) -> Vec<f64> {
    let (a, b) = match sym {
        Symmetry::Rotational => return vec![0.0],
        Symmetry::Quadrant => (0.0, 90.0),
        Symmetry::BilateralC0 => (0.0, 180.0),
        Symmetry::BilateralC90 => (90.0, 270.0),
        Symmetry::Full => (0.0, 360.0),
    };
    let n = ((b - a) / 30.0) as usize;
    (0..=n).map(|k| a + 30.0 * k as f64).collect()
}

/// An IES file of `f_sym` on the planes `sym` stores, candela values
/// divided by `mult` (the file's multiplier restores them).
fn ies_text(sym: Symmetry, mult: f64, tilt: &str) -> String {
    let hs = planes(sym);
    let mut s = format!(
        "IESNA:LM-63-2002\n[TEST] unit\n[MANUFAC] gloam\n{tilt}\n1 1000 {mult} {} {} 1 2 0 0 0\n1.0 1.0 10\n{}\n{}\n",
        GAMMAS.len(),
        hs.len(),
        join(&GAMMAS),
        join(&hs)
    );
    for &c in &hs {
        let row: Vec<f64> = GAMMAS.iter().map(|&g| f_sym(sym, g, c) / mult).collect();
        s += &join(&row);
        s += "\n";
    }
    s
}

/// The same distribution as EULUMDAT: 12 C-planes every 30°, intensities
/// in cd/klm of a 2000 lm lamp.
fn ldt_text(sym: Symmetry) -> String {
    let isym = match sym {
        Symmetry::Full => 0,
        Symmetry::Rotational => 1,
        Symmetry::BilateralC0 => 2,
        Symmetry::BilateralC90 => 3,
        Symmetry::Quadrant => 4,
    };
    let mc = 12usize;
    let c_all: Vec<f64> = (0..mc).map(|k| 30.0 * k as f64).collect();
    let stored: Vec<f64> = match sym {
        Symmetry::Full => c_all.clone(),
        Symmetry::Rotational => vec![0.0],
        Symmetry::BilateralC0 => (0..=6).map(|k| 30.0 * k as f64).collect(),
        Symmetry::BilateralC90 => (9..=15).map(|k| (30.0 * k as f64) % 360.0).collect(),
        Symmetry::Quadrant => (0..=3).map(|k| 30.0 * k as f64).collect(),
    };
    let mut lines: Vec<String> = vec![
        "gloam test".into(),
        "1".into(),
        isym.to_string(),
        mc.to_string(),
        "30".into(),
        GAMMAS.len().to_string(),
        "0".into(),
    ];
    lines.extend(["report", "lum", "no", "file.ldt", "date"].map(String::from));
    lines.extend((13..=22).map(|_| "0".to_string()));
    lines.push("80,5".into()); // LORL, with a decimal comma
    lines.push("1".into()); // conversion factor
    lines.push("0".into()); // tilt during measurement
    lines.push("1".into()); // one lamp set
    lines.extend(["1", "LED", "2000", "3000K", "80", "20"].map(String::from));
    lines.extend((0..10).map(|_| "0.5".to_string()));
    lines.extend(c_all.iter().map(|c| format!("{c}")));
    lines.extend(GAMMAS.iter().map(|g| format!("{g}")));
    for &c in &stored {
        for &g in &GAMMAS {
            lines.push(format!("{}", f_sym(sym, g, c) / 2.0));
        }
    }
    lines.join("\r\n") + "\r\n"
}

const ALL: [Symmetry; 5] = [
    Symmetry::Rotational,
    Symmetry::Quadrant,
    Symmetry::BilateralC0,
    Symmetry::BilateralC90,
    Symmetry::Full,
];

#[test]
fn ies_symmetries_fold_to_the_full_distribution() {
    for sym in ALL {
        let p = Photometry::parse_ies(&ies_text(sym, 2.5, "TILT=NONE"), "t.ies").unwrap();
        assert_eq!(p.symmetry, sym);
        // At every node of the full 30° grid the folded table is exact.
        for &g in &GAMMAS {
            for k in 0..12 {
                let c = 30.0 * k as f64;
                let want = f_sym(sym, g, c);
                let got = p.candela_at(g, c);
                assert!(
                    (got - want).abs() <= 1e-9 * want,
                    "{sym:?} γ {g} C {c}: {got} vs {want}"
                );
            }
        }
        assert_eq!(p.header_lumens, Some(1000.0));
    }
}

#[test]
fn ldt_and_ies_of_one_distribution_give_one_table() {
    for sym in ALL {
        let i = Photometry::parse_ies(&ies_text(sym, 1.0, "TILT=NONE"), "t.ies").unwrap();
        let l = Photometry::parse_ldt(&ldt_text(sym), "t.ldt").unwrap();
        assert_eq!(l.symmetry, sym, "{sym:?}");
        assert_eq!(l.vertical_deg, i.vertical_deg, "{sym:?}");
        assert_eq!(l.horizontal_deg, i.horizontal_deg, "{sym:?}");
        for (a, b) in l.candela.iter().zip(&i.candela) {
            assert!((a - b).abs() <= 1e-12 * b, "{sym:?}: {a} vs {b}");
        }
        // 2000 lm × 80.5 %.
        assert!((l.header_lumens.unwrap() - 1610.0).abs() < 1e-9);
        for g in [0.0, 7.0, 44.0, 100.0, 179.0] {
            for c in [0.0, 13.0, 95.0, 181.0, 269.0, 300.0, 359.9] {
                let (a, b) = (l.candela_at(g, c), i.candela_at(g, c));
                assert!((a - b).abs() <= 1e-12 * b, "{sym:?} {g} {c}: {a} vs {b}");
            }
        }
    }
}

#[test]
fn interpolation_is_bilinear_between_nodes() {
    let p = Photometry::parse_ies(&ies_text(Symmetry::Full, 1.0, "TILT=NONE"), "t.ies").unwrap();
    let (g0, g1, c0, c1) = (30.0, 60.0, 90.0, 120.0);
    let (tg, tc) = (0.25, 0.6);
    let v = |g, c| f(g, c);
    let want = (1.0 - tc) * ((1.0 - tg) * v(g0, c0) + tg * v(g1, c0))
        + tc * ((1.0 - tg) * v(g0, c1) + tg * v(g1, c1));
    let got = p.candela_at(g0 + tg * (g1 - g0), c0 + tc * (c1 - c0));
    assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    // The wrap from 330° to 360° = 0°.
    let want = 0.5 * (f(45.0, 330.0) + f(45.0, 0.0));
    let got = p.candela_at(45.0, 345.0);
    assert!((got - 0.5 * (p.candela_at(30.0, 345.0) + p.candela_at(60.0, 345.0))).abs() < 1e-9);
    let _ = want;
    // Beyond the table's vertical range: nothing.
    let q = Photometry::parse_ies(
        "IESNA91\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 1\n0 90\n0\n5 5\n",
        "t.ies",
    )
    .unwrap();
    assert_eq!(q.candela_at(90.5, 0.0), 0.0);
    assert_eq!(q.candela_at(45.0, 77.0), 5.0);
    assert_eq!(q.header_lumens, None);
    assert_eq!(q.support_deg(), 90.0);
}

/// I = I0 (1 + cos γ) on [0°, 180°], rotationally symmetric, has flux
/// 4π I0 exactly; a 1° grid of it, integrated as the bilinear table it is,
/// is within (Δγ)²/8 · max|f''|/f of that.
#[test]
fn flux_of_a_closed_form_distribution() {
    let n = 181;
    let g: Vec<f64> = (0..n).map(|k| k as f64).collect();
    let vals: Vec<f64> = g
        .iter()
        .map(|x| 50.0 * (1.0 + x.to_radians().cos()))
        .collect();
    let text = format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 {n} 1 1 2 0 0 0\n1 1 1\n{}\n0\n{}\n",
        join(&g),
        join(&vals)
    );
    let p = Photometry::parse_ies(&text, "t.ies").unwrap();
    let exact = 4.0 * std::f64::consts::PI * 50.0;
    let rel = (p.flux_lm() - exact).abs() / exact;
    assert!(rel < 1e-4, "{} vs {exact}: {rel}", p.flux_lm());
    // An independent quadrature (midpoint in cos γ and C over candela_at).
    let (ng, nc) = (2000, 16);
    let mut sum = 0.0;
    for i in 0..ng {
        let mu = -1.0 + (i as f64 + 0.5) * 2.0 / ng as f64;
        for j in 0..nc {
            let c = (j as f64 + 0.5) * 360.0 / nc as f64;
            sum += p.candela_at(mu.acos().to_degrees(), c);
        }
    }
    let quad = sum * (2.0 / ng as f64) * (2.0 * std::f64::consts::PI / nc as f64);
    assert!(
        (quad - p.flux_lm()).abs() < 1e-5 * exact,
        "{quad} vs {}",
        p.flux_lm()
    );
}

#[test]
fn tilt_include_is_read_and_interpolated() {
    let tilt = "TILT=INCLUDE\n1\n3\n0 45 90\n1.0 0.8 0.5";
    let p = Photometry::parse_ies(&ies_text(Symmetry::Rotational, 1.0, tilt), "t.ies").unwrap();
    let t = p.tilt.as_ref().unwrap();
    assert_eq!(t.geometry, 1);
    assert!((t.factor(22.5) - 0.9).abs() < 1e-12);
    assert!((t.factor(67.5) - 0.65).abs() < 1e-12);
    assert_eq!(t.factor(120.0), 0.5);
    // The candela multiplier, ballast factor and ballast-lamp factor all
    // multiply.
    let text = ies_text(Symmetry::Rotational, 4.0, "TILT=NONE").replace("1.0 1.0 10", "0.5 0.5 10");
    let p = Photometry::parse_ies(&text, "t.ies").unwrap();
    let want = 0.25 * f(0.0, 0.0);
    assert!((p.candela_at(0.0, 0.0) - want).abs() < 1e-9 * want);
}

fn ies_err(text: &str) -> String {
    match Photometry::parse_ies(text, "bad.ies") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_ies_files_are_refused_by_line_and_field() {
    let good = ies_text(Symmetry::Quadrant, 1.0, "TILT=NONE");
    let cases: Vec<(String, &str)> = vec![
        (
            good.replace("TILT=NONE", "TILT=lamp.tlt"),
            "bad.ies:4: TILT: TILT=lamp.tlt",
        ),
        (good.replace("TILT=NONE\n", ""), "TILT: no `TILT=` line"),
        (
            good.replace("1 1000 1 7 4", "1 1000 1 -7 4"),
            "number of vertical angles: -7 must be a whole number",
        ),
        (
            good.replace("1 1000 1 7 4", "1 1000 1 7 4.5"),
            "number of horizontal angles: 4.5 must be a whole",
        ),
        (
            good.replace("1 1000 1 7 4", "1 1000 1 7 99999"),
            "candela values: the header promises",
        ),
        (
            good.replace("1 1000 1 7 4", "1 1000 1 100000 100000"),
            "is more than the limit",
        ),
        (
            good.replace("1 1000 1 7 4", "1 1000 1 7 4000000"),
            "more than the limit of 100000",
        ),
        (
            good.replace("0 15 30 60", "0 30 15 60"),
            "bad.ies:7: vertical angles: angles must increase",
        ),
        (
            good.replace("0 15 30 60", "0 15 NaN 60"),
            "vertical angles: NaN is not a finite number",
        ),
        (
            good.replace("0 15 30 60", "0 15 x 60"),
            "vertical angles: 'x' is not a number",
        ),
        (
            good.replace("\n0 30 60 90\n", "\n0 30 60 80\n"),
            "horizontal angles: 0° to 80°",
        ),
        (
            good.replace("1 1000 1 7 4 1", "1 1000 1 7 4 2"),
            "photometric type: 2 (type B",
        ),
        (
            good.replace("1 1000 1", "1 0 1"),
            "lumens per lamp: 0 must be > 0, or −1",
        ),
        (
            good.replace("1 1000 1", "1 1000 -1"),
            "candela multiplier: -1 must be > 0",
        ),
        (
            good.replace("1.0 1.0 10", "0 1.0 10"),
            "ballast factor: 0 must be > 0",
        ),
        (
            good.replace("1 1000 1 7 4", "1 1000 1e-320 7 4"),
            "bad.ies:5: candela multiplier: 1e-320 is below 1e-12",
        ),
        (
            good.replace("1.0 1.0 10", "1.0 5e-13 10"),
            "bad.ies:6: ballast-lamp photometric factor: 5e-13 is below 1e-12",
        ),
        (
            good.clone() + "77 88\n99\n",
            "bad.ies:13: candela values: 3 numbers after the candela table: the angle counts (line 5) say 7 × 4 values",
        ),
        (
            // One horizontal angle too few: the table reads shifted and
            // the last plane is left over.
            "IESNA:LM-63-2002\n[TEST] x\nTILT=NONE\n1 -1 1 3 1 1 1 0.5 0.5 0\n1 1 100\n0 45 90\n0 90\n1000 500 0\n1000 500 0\n".to_string(),
            "bad.ies:8: candela values: 4 numbers after the candela table: the angle counts (line 4) say 3 × 1 values",
        ),
        (
            good[..good.len() - 20].to_string(),
            "the file ends here (truncated?)",
        ),
        (
            good.replace("TILT=NONE", "TILT=INCLUDE\n1\n2\n0 90\n1 -1"),
            "tilt multiplying factors: -1e0 must be in 0..=10",
        ),
        (
            good.replace("TILT=NONE", "TILT=INCLUDE\n1\n2\n0 90\n1 1e300"),
            "tilt multiplying factors: 1e300 must be in 0..=10",
        ),
        (
            good.replace("TILT=NONE", "TILT=INCLUDE\n1\n2\n0 90\nNaN 1"),
            "tilt multiplying factors",
        ),
        (
            good.replace("TILT=NONE", "TILT=INCLUDE\n7\n2\n0 90\n1 1"),
            "lamp-to-luminaire geometry: 7",
        ),
    ];
    for (text, want) in cases {
        let e = ies_err(&text);
        assert!(e.contains(want), "{e}\n  should contain: {want}");
        assert!(e.starts_with("bad.ies:"), "{e}");
    }
    // Negative and zero candela, every value zero.
    let mut neg = good.clone();
    neg.truncate(neg.trim_end().rfind(' ').unwrap());
    neg += " -3\n";
    assert!(ies_err(&neg).contains("candela values: candela value -3"));
}

#[test]
fn every_truncation_and_byte_flip_is_an_error_not_a_panic() {
    for text in [
        ies_text(
            Symmetry::BilateralC90,
            1.0,
            "TILT=INCLUDE\n1\n2\n0 90\n1 0.5",
        ),
        ldt_text(Symmetry::BilateralC90),
    ] {
        let ldt = !text.starts_with("IESNA");
        let parse = |t: &str| {
            if ldt {
                Photometry::parse_ldt(t, "x.ldt")
            } else {
                Photometry::parse_ies(t, "x.ies")
            }
        };
        assert!(parse(&text).is_ok());
        for cut in 0..text.len() {
            if text.is_char_boundary(cut) {
                let _ = parse(&text[..cut]);
            }
        }
        for (i, c) in text.char_indices() {
            for r in ["-", "9", "e", "\n", " ", "1e300", "nan"] {
                let mut t = text.clone();
                t.replace_range(i..i + c.len_utf8(), r);
                if let Ok(p) = parse(&t) {
                    assert!(p.max_candela > 0.0 && p.max_candela.is_finite());
                    assert!(p.candela.iter().all(|v| v.is_finite() && *v >= 0.0));
                }
            }
        }
    }
}

#[test]
fn trailing_blank_lines_and_a_dos_eof_mark_are_accepted() {
    let ldt = ldt_text(Symmetry::Quadrant);
    for t in [ldt.clone() + "\r\n  \r\n", ldt.clone() + "\u{1a}"] {
        assert!(Photometry::parse_ldt(&t, "x.ldt").is_ok());
    }
    let ies = ies_text(Symmetry::Quadrant, 1.0, "TILT=NONE");
    for t in [ies.clone() + "\n \n", ies.clone() + "\u{1a}"] {
        assert!(Photometry::parse_ies(&t, "x.ies").is_ok());
    }
}

#[test]
fn bad_ldt_files_are_refused_by_line_and_field() {
    let good = ldt_text(Symmetry::Quadrant);
    let set = |line: usize, v: &str| {
        let mut l: Vec<&str> = good.split("\r\n").collect();
        l[line - 1] = v;
        l.join("\r\n")
    };
    let cases = [
        (
            set(3, "7"),
            "bad.ldt:3: Isym (symmetry indicator): 7 must be 0, 1, 2, 3 or 4",
        ),
        (
            set(4, "-12"),
            "bad.ldt:4: Mc (number of C-planes): -12 must be a whole number",
        ),
        (set(4, "10"), "cannot be split by symmetry"),
        (set(6, "99999"), "truncated?"),
        (
            set(6, "nan"),
            "bad.ldt:6: Ng (number of intensities per C-plane): NaN is not a finite",
        ),
        (
            set(23, "180"),
            "bad.ldt:23: LORL (light output ratio): 180 % must be in 0..=100",
        ),
        (
            set(26, "0"),
            "bad.ldt:26: n (number of lamp sets): 0 must be a whole number",
        ),
        (
            set(29, "0"),
            "bad.ldt:29: total luminous flux of lamps (set 1): must be non-zero",
        ),
        (
            set(46, "45"),
            "bad.ldt:46: C-plane angles: angles must increase",
        ),
        (
            set(64, "-5"),
            "bad.ldt:64: luminous intensity (cd/klm): candela value -10 (entry 3)",
        ),
        (good[..good.len() - 10].to_string(), "truncated?"),
        (
            good.clone() + "\r\n1\r\n2\r\n",
            "bad.ldt:91: luminous intensity distribution: 2 non-empty lines after the intensity table, which ends at line 89",
        ),
    ];
    for (text, want) in cases {
        let e = match Photometry::parse_ldt(&text, "bad.ldt") {
            Ok(_) => panic!("accepted ({want})"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(want), "{e}\n  should contain: {want}");
    }
}
