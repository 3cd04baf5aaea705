//! `gloam sweep collect`: every task's figures into one table, and plots.
//!
//! `results.csv` and `results.json` hold one row per task, in task order:
//! `index`, `id`, one column per axis, `status`, `seed`, every figure any
//! task reported (sorted by name; empty/null where a task has none), the
//! `outputs_sha256` of the task's output files, and `error`. Nothing in
//! them depends on where or when a task ran, so a Slurm run and a local
//! run of one sweep give identical files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use gloam_calib::plot::{Mark, Scale, Series, xy_plot_scaled};

use gloam_pipeline::output::write_atomic;

use crate::run::{SweepDir, TaskRecord, sha256_hex};

/// What `collect` wrote.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Collected {
    pub rows: usize,
    pub done: usize,
    pub failed: usize,
    pub missing: usize,
    pub files: Vec<PathBuf>,
}

fn outputs_hash(r: &TaskRecord) -> String {
    let text: String = r
        .outputs
        .iter()
        .map(|(f, h)| format!("{h}  {f}\n"))
        .collect();
    sha256_hex(text.as_bytes())
}

/// A scene's short name: its directory for `…/NAME/scene.toml`, else its file name.
fn scene_label(s: &str) -> String {
    let p = std::path::Path::new(s);
    let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
    match (name.as_deref(), p.parent().and_then(|d| d.file_name())) {
        (Some("scene.toml"), Some(dir)) => dir.to_string_lossy().into_owned(),
        (Some(n), _) => n.trim_end_matches(".toml").to_string(),
        _ => s.to_string(),
    }
}

fn slug(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    while out.contains("--") {
        out = out.replace("--", "-");
    }
    let out = out.trim_matches('-');
    let out: String = out
        .chars()
        .rev()
        .take(80)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    if out.is_empty() { "all".into() } else { out }
}

/// Why `results.csv`, `results.json` or `figures/` was not written, naming
/// the file or directory.
#[derive(Debug, thiserror::Error)]
pub enum CollectError {
    #[error("writing {}", path.display())]
    Csv {
        path: PathBuf,
        #[source]
        source: csv::Error,
    },
    #[error("writing {}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error(transparent)]
    Write(#[from] gloam_pipeline::output::OutputError),
    #[error("creating a temporary directory in {}", dir.display())]
    TempDir {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("plotting {name}")]
    Plot {
        name: String,
        /// Boxed: the calibration error is large.
        #[source]
        source: Box<gloam_calib::CalibError>,
    },
    #[error("replacing {}", path.display())]
    Replace {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("renaming into {}", path.display())]
    Rename {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Writes `DIR/results.csv`, `DIR/results.json` and, when the sweep has a
/// gain axis and camera figures, `DIR/figures/` (mean DN and SNR against
/// gain, one plot per scene, one line per camera).
pub fn collect(sd: &SweepDir) -> Result<Collected, CollectError> {
    let sweep = &sd.sweep;
    let records: Vec<Option<TaskRecord>> = sweep.tasks.iter().map(|t| sd.record(t.index)).collect();
    let figure_names: BTreeSet<String> = records
        .iter()
        .flatten()
        .flat_map(|r| r.figures.keys().cloned())
        .collect();
    let axis_names: Vec<String> = sweep.axes.iter().map(|a| a.name.clone()).collect();
    let mut columns: Vec<String> = vec!["index".into(), "id".into()];
    columns.extend(axis_names.iter().cloned());
    // `noise_seed`, not `seed`: a `seed` axis made two columns of one name
    // (and the JSON row kept only the derived one).
    columns.extend(["status".to_string(), "noise_seed".to_string()]);
    columns.extend(figure_names.iter().cloned());
    columns.extend(["outputs_sha256".to_string(), "error".to_string()]);

    let mut files = vec![sd.dir.join("results.csv"), sd.dir.join("results.json")];
    let csv_error = |source| CollectError::Csv {
        path: files[0].clone(),
        source,
    };
    let mut csv_w = csv::Writer::from_writer(Vec::new());
    csv_w.write_record(&columns).map_err(csv_error)?;
    let mut json_rows = Vec::new();
    let (mut done, mut failed, mut missing) = (0, 0, 0);
    for (t, r) in sweep.tasks.iter().zip(&records) {
        let mut row: Vec<String> = vec![t.index.to_string(), t.id.clone()];
        let mut obj = serde_json::Map::new();
        obj.insert("index".into(), t.index.into());
        obj.insert("id".into(), t.id.clone().into());
        for (k, v) in &t.axes {
            row.push(v.clone());
            obj.insert(k.clone(), v.clone().into());
        }
        let status = match r {
            Some(r) if sd.is_done(t.index) => {
                done += 1;
                let _ = r;
                "done"
            }
            Some(r) if r.status == crate::run::Status::Failed => {
                failed += 1;
                "failed"
            }
            Some(_) => {
                missing += 1;
                "changed"
            }
            None => {
                missing += 1;
                "pending"
            }
        };
        row.push(status.into());
        row.push(t.seed.to_string());
        obj.insert("status".into(), status.into());
        obj.insert("noise_seed".into(), t.seed.into());
        for f in &figure_names {
            let v = r.as_ref().and_then(|r| r.figures.get(f).copied().flatten());
            row.push(v.map(|x| format!("{x:e}")).unwrap_or_default());
            obj.insert(f.clone(), v.map_or(serde_json::Value::Null, Into::into));
        }
        let oh = r
            .as_ref()
            .filter(|r| r.status == crate::run::Status::Done)
            .map(outputs_hash)
            .unwrap_or_default();
        row.push(oh.clone());
        obj.insert("outputs_sha256".into(), oh.into());
        let err = r.as_ref().and_then(|r| r.error.clone()).unwrap_or_default();
        row.push(err.clone());
        obj.insert("error".into(), err.into());
        csv_w.write_record(&row).map_err(csv_error)?;
        json_rows.push(serde_json::Value::Object(obj));
    }
    let csv_bytes = csv_w
        .into_inner()
        .map_err(|e| csv_error(e.into_error().into()))?;
    let json = serde_json::json!({
        "format": "gloam-sweep-results/1",
        "columns": columns,
        "rows": json_rows,
    });
    write_atomic(&files[0], &csv_bytes)?;
    let text = serde_json::to_string_pretty(&json).map_err(|source| CollectError::Json {
        path: files[1].clone(),
        source,
    })?;
    write_atomic(&files[1], text.as_bytes())?;
    files.extend(plots(sd, &records)?);
    Ok(Collected {
        rows: sweep.tasks.len(),
        done,
        failed,
        missing,
        files,
    })
}

/// Done tasks' figures summed per scene → camera → gain bits: (sum mean
/// DN, count, sum SNR, count).
type GainFigures = BTreeMap<String, BTreeMap<String, BTreeMap<u64, [f64; 4]>>>;

/// The mean DN and SNR of the done tasks, summed by scene, camera and
/// gain (a task without a gain axis value is left out).
fn gain_figures(sd: &SweepDir, records: &[Option<TaskRecord>]) -> GainFigures {
    let mut acc: GainFigures = BTreeMap::new();
    for (t, r) in sd.sweep.tasks.iter().zip(records) {
        let (Some(r), Some(g)) = (r, t.gain()) else {
            continue;
        };
        if r.status != crate::run::Status::Done {
            continue;
        }
        let scene = t
            .text("scene")
            .map_or_else(|| "uniform stimulus".into(), |s| scene_label(&s));
        let cam = t.text("sensor").unwrap_or_else(|| "camera".into());
        let e = acc
            .entry(scene)
            .or_default()
            .entry(cam)
            .or_default()
            .entry(g.to_bits())
            .or_insert([0.0; 4]);
        if let Some(Some(v)) = r.figures.get("mean_dn") {
            e[0] += v;
            e[1] += 1.0;
        }
        if let Some(Some(v)) = r.figures.get("snr") {
            e[2] += v;
            e[3] += 1.0;
        }
    }
    acc
}

/// Mean DN and SNR against gain, per scene, one line per camera (the mean
/// over the tasks' other axes at each gain).
fn plots(sd: &SweepDir, records: &[Option<TaskRecord>]) -> Result<Vec<PathBuf>, CollectError> {
    let has_gain_axis = sd.sweep.axes.iter().any(|a| a.name == "gain");
    if !has_gain_axis {
        return Ok(Vec::new());
    }
    let acc = gain_figures(sd, records);
    if acc
        .values()
        .all(|c| c.values().all(|g| g.values().all(|e| e[1] == 0.0)))
    {
        return Ok(Vec::new());
    }
    let tmp = tempfile::Builder::new()
        .prefix(".figures-")
        .tempdir_in(&sd.dir)
        .map_err(|source| CollectError::TempDir {
            dir: sd.dir.clone(),
            source,
        })?;
    let mut names = Vec::new();
    for (scene, cams) in &acc {
        let gain_scale = if cams
            .values()
            .all(|g| g.keys().all(|&b| f64::from_bits(b) > 0.0))
        {
            Scale::Log10
        } else {
            Scale::Linear
        };
        for (fig, (si, ni), label) in [
            ("mean_dn", (0, 1), "mean DN"),
            ("snr", (2, 3), "SNR (signal / temporal noise)"),
        ] {
            let series: Vec<Series> = cams
                .iter()
                .map(|(cam, gains)| {
                    let mut pts: Vec<(f64, f64)> = gains
                        .iter()
                        .filter(|(_, e)| e[ni] > 0.0)
                        .map(|(&b, e)| (f64::from_bits(b), e[si] / e[ni]))
                        .collect();
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    Series::new(cam, pts, Mark::LinePoints)
                })
                .filter(|s| !s.points.is_empty())
                .collect();
            if series.is_empty() {
                continue;
            }
            let name = format!("{}-{fig}.png", slug(scene));
            xy_plot_scaled(
                &tmp.path().join(&name),
                &format!("{label} against gain: {scene}"),
                ("gain", gain_scale),
                (label, Scale::Linear),
                &series,
            )
            .map_err(|source| CollectError::Plot {
                name: name.clone(),
                source: Box::new(source),
            })?;
            names.push(name);
        }
    }
    // The plots are published as one directory.
    let dest = sd.dir.join("figures");
    if dest.exists() {
        std::fs::remove_dir_all(&dest).map_err(|source| CollectError::Replace {
            path: dest.clone(),
            source,
        })?;
    }
    let kept = tmp.keep();
    std::fs::rename(&kept, &dest).map_err(|source| CollectError::Rename {
        path: dest.clone(),
        source,
    })?;
    Ok(names.into_iter().map(|n| dest.join(n)).collect())
}
