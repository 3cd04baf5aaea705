//! What only a task used to check, checked when the sweep is planned: each
//! render's scene with its dotted overrides, each camera task's sensor,
//! gain and frames. A missing scene, a `camera.width = 0` or a gain
//! outside the camera's range was planned, written into `sweep.sbatch`
//! and failed task by task (on the cluster, after submission); now the
//! plan is refused naming the sweep file and the task.

use std::collections::{BTreeMap, BTreeSet};

use crate::spec::{Flow, Sweep, Task};

/// A task the plan refuses, with the reason the task would have failed.
#[derive(Debug, thiserror::Error)]
#[error("{}: task {index} ({describe})", path.display())]
pub struct PreflightError {
    pub path: std::path::PathBuf,
    pub index: usize,
    pub describe: String,
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

/// Loads each distinct scene (with its overrides) and resolves each
/// distinct sensor once, checking every task's gain and frames against its
/// camera; reads nothing into the plan's provenance (the tasks record what
/// they read).
pub fn check(sweep: &Sweep) -> Result<(), PreflightError> {
    let off = gloam_io::ReadLog::off();
    let mut scenes = BTreeSet::new();
    let mut geometry = BTreeSet::new();
    let mut sensors = BTreeMap::new();
    for task in &sweep.tasks {
        let refuse = |source: Box<dyn std::error::Error + Send + Sync>| PreflightError {
            path: sweep.path.clone(),
            index: task.index,
            describe: task.describe(),
            source,
        };
        if task.flow() == Flow::Render && scenes.insert(scene_key(task, false)) {
            // A task differing from a loaded one only in `camera.*` keys: its
            // camera alone is checked (the whole scene when that check fails,
            // for the build's own message).
            let cheap = !geometry.insert(scene_key(task, true)) && sweep.check_camera(task).is_ok();
            if !cheap {
                sweep.load_scene(task, &off).map_err(|e| refuse(e.into()))?;
            }
        }
        let Some(name) = sweep.sensor(task) else {
            continue;
        };
        if !sensors.contains_key(&name) {
            let s = gloam_pipeline::resolve_sensor(&name, &off).map_err(|e| refuse(e.into()))?;
            sensors.insert(name.clone(), s);
        }
        gloam_pipeline::check_options(&sensors[&name], task.gain(), task.frames())
            .map_err(|e| refuse(e.into()))?;
    }
    Ok(())
}

/// The scene and its overrides: tasks that share them load one scene
/// (`beside_camera`: only the overrides outside `camera.*`).
fn scene_key(task: &Task, beside_camera: bool) -> String {
    let mut key = task.text("scene").unwrap_or_default();
    for (k, v) in task.scene_overrides() {
        if beside_camera && k.starts_with("camera.") {
            continue;
        }
        key.push_str(&format!("\n{k}={v}"));
    }
    key
}
