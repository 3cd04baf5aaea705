//! Slurm: the array-job script, submitting it, and asking Slurm about it.
//!
//! One array index per chunk (the tasks that share a render), each running
//! `gloam sweep run DIR --chunk $SLURM_ARRAY_TASK_ID`; Slurm does the
//! scheduling, gloam only keeps the records.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use gloam_pipeline::output::{OutputError, write_atomic};
use serde::{Deserialize, Serialize};

/// `sbatch` options from the command line.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct SlurmOptions {
    pub partition: Option<String>,
    /// Slurm's time format (`MM`, `HH:MM:SS`, `D-HH`…).
    pub time: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// At most this many array tasks at once (`--array=…%K`).
    pub max_parallel: Option<u32>,
    /// `--jobs`: tasks at once within each array task's chunk, passed to
    /// `sweep run` (the script dropped it).
    #[serde(default)]
    pub jobs: Option<usize>,
}

/// `DIR/slurm.json`: the submitted job.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Submission {
    pub job_id: String,
    pub script: String,
    pub array_size: usize,
    pub options: SlurmOptions,
}

pub const SCRIPT_FILE: &str = "sweep.sbatch";
pub const SUBMISSION_FILE: &str = "slurm.json";

/// Single-quoted for sh.
fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// Why an array job was not scripted or submitted, naming the option,
/// path or command at fault.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    #[error("the sweep has no tasks")]
    NoTasks,
    #[error("{option} must be at least 1")]
    NotPositive { option: &'static str },
    #[error(
        "{option} '{value}' has characters Slurm does not take there (letters, digits, - _ : . , + only)"
    )]
    BadWord { option: &'static str, value: String },
    #[error(
        "--time '{value}' is not a Slurm time limit (MINUTES, MM:SS, HH:MM:SS, DAYS-HH, DAYS-HH:MM, DAYS-HH:MM:SS or UNLIMITED)"
    )]
    BadTime { value: String },
    #[error("the {what}'s path is not UTF-8")]
    NotUtf8 { what: &'static str },
    #[error("paths with newlines cannot go into an sbatch script")]
    Newline,
    #[error("creating {}", path.display())]
    CreateDir {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Write(#[from] OutputError),
    #[error("writing {}", path.display())]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("running sbatch (is Slurm installed and on PATH? --dry-run only writes the script)")]
    Spawn(#[source] std::io::Error),
    #[error("sbatch failed ({status}): {stderr}")]
    Sbatch {
        status: std::process::ExitStatus,
        stderr: String,
    },
    #[error("sbatch printed no job id: '{0}'")]
    NoJobId(String),
}

fn check_word(option: &'static str, v: &str) -> Result<(), SlurmError> {
    let ok = |c: char| c.is_ascii_alphanumeric() || "-_:.,+".contains(c);
    if v.is_empty() || !v.chars().all(ok) {
        let value = v.to_string();
        return Err(SlurmError::BadWord { option, value });
    }
    Ok(())
}

/// `Ok` when `t` is one of sbatch's time-limit forms: `--time abc` was
/// written into the script, to be refused by Slurm at submission (or,
/// with `--dry-run`, never).
fn check_time(t: &str) -> Result<(), SlurmError> {
    let digits = |p: &str| !p.is_empty() && p.len() <= 9 && p.bytes().all(|b| b.is_ascii_digit());
    let fields = |p: &str, most: usize| {
        let f: Vec<&str> = p.split(':').collect();
        f.len() <= most && f.iter().all(|x| digits(x))
    };
    let ok = ["unlimited", "infinite"].contains(&t.to_ascii_lowercase().as_str())
        || match t.split_once('-') {
            Some((days, rest)) => digits(days) && fields(rest, 3),
            None => fields(t, 3),
        };
    match ok {
        true => Ok(()),
        false => Err(SlurmError::BadTime {
            value: t.to_string(),
        }),
    }
}

/// `Ok` when `n` (the value of `option`) is at least 1.
fn check_positive(option: &'static str, n: u32) -> Result<(), SlurmError> {
    match n {
        0 => Err(SlurmError::NotPositive { option }),
        _ => Ok(()),
    }
}

/// The array-job script for `chunks` array indices of the sweep in `dir`
/// (absolute), run by the `gloam` binary at `exe`.
pub fn script(
    dir: &Path,
    exe: &Path,
    chunks: usize,
    o: &SlurmOptions,
) -> Result<String, SlurmError> {
    if chunks == 0 {
        return Err(SlurmError::NoTasks);
    }
    let dir_s = dir.to_str().ok_or(SlurmError::NotUtf8 {
        what: "sweep directory",
    })?;
    let exe_s = exe.to_str().ok_or(SlurmError::NotUtf8 {
        what: "gloam binary",
    })?;
    if dir_s.contains('\n') || exe_s.contains('\n') {
        return Err(SlurmError::Newline);
    }
    let mut s = String::from("#!/bin/sh\n");
    s.push_str("# Written by `gloam sweep --slurm`: one array index per chunk of tasks.\n");
    s.push_str("#SBATCH --job-name=gloam-sweep\n");
    let mut array = format!("0-{}", chunks - 1);
    if let Some(k) = o.max_parallel {
        check_positive("--max-parallel", k)?;
        array.push_str(&format!("%{k}"));
    }
    s.push_str(&format!("#SBATCH --array={array}\n"));
    // #SBATCH lines are not shell: Slurm reads the path up to the line's end.
    s.push_str(&format!("#SBATCH --output={dir_s}/slurm/%A_%a.out\n"));
    if let Some(p) = &o.partition {
        check_word("--partition", p)?;
        s.push_str(&format!("#SBATCH --partition={p}\n"));
    }
    if let Some(t) = &o.time {
        check_word("--time", t)?;
        check_time(t)?;
        s.push_str(&format!("#SBATCH --time={t}\n"));
    }
    if let Some(c) = o.cpus_per_task {
        check_positive("--cpus-per-task", c)?;
        s.push_str(&format!("#SBATCH --cpus-per-task={c}\n"));
        s.push_str(&format!("export RAYON_NUM_THREADS={c}\n"));
    }
    s.push_str("set -eu\n");
    let jobs = o.jobs.map(|j| format!(" --jobs {j}")).unwrap_or_default();
    s.push_str(&format!(
        "exec {} sweep run {} --chunk \"$SLURM_ARRAY_TASK_ID\"{jobs}\n",
        sh_quote(exe_s),
        sh_quote(dir_s)
    ));
    Ok(s)
}

/// Writes `DIR/sweep.sbatch` for the sweep in `dir` (absolute) with
/// `chunks` array indices, and `DIR/slurm/` for the array tasks' logs;
/// returns the script's path.
pub fn write_script(
    dir: &Path,
    exe: &Path,
    chunks: usize,
    o: &SlurmOptions,
) -> Result<PathBuf, SlurmError> {
    let text = script(dir, exe, chunks, o)?;
    let path = dir.join(SCRIPT_FILE);
    write_atomic(&path, text.as_bytes())?;
    let logs = dir.join("slurm");
    std::fs::create_dir_all(&logs)
        .map_err(|source| SlurmError::CreateDir { path: logs, source })?;
    Ok(path)
}

/// Submits the array job `script` of `array_size` indices and records it
/// in `DIR/slurm.json` (`dir` holds the script).
pub fn submit_and_record(
    dir: &Path,
    script: &Path,
    array_size: usize,
    options: SlurmOptions,
) -> Result<Submission, SlurmError> {
    let job_id = submit(script)?;
    let sub = Submission {
        job_id,
        script: script.display().to_string(),
        array_size,
        options,
    };
    let path = dir.join(SUBMISSION_FILE);
    let text = serde_json::to_string_pretty(&sub).map_err(|source| SlurmError::Json {
        path: path.clone(),
        source,
    })?;
    write_atomic(&path, text.as_bytes())?;
    Ok(sub)
}

/// The job submitted for the sweep in `dir`, if one was (and its record
/// reads).
pub fn read_submission(dir: &Path) -> Option<Submission> {
    // The sweep directory's own record, not an input.
    let own = gloam_io::ReadLog::off();
    gloam_io::read_text(
        &dir.join(SUBMISSION_FILE),
        gloam_io::MAX_TEXT_FILE_BYTES,
        &own,
    )
    .ok()
    .and_then(|t| serde_json::from_str(&t).ok())
}

/// Submits `script` with `sbatch --parsable`; returns the job id.
pub fn submit(script: &Path) -> Result<String, SlurmError> {
    let out = Command::new("sbatch")
        .arg("--parsable")
        .arg(script)
        .output()
        .map_err(SlurmError::Spawn)?;
    if !out.status.success() {
        return Err(SlurmError::Sbatch {
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).trim().to_string(),
        });
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // `JOBID` or `JOBID;CLUSTER`.
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(SlurmError::NoJobId(text.trim().to_string()));
    }
    Ok(id)
}

/// What Slurm says about a job's array tasks.
#[derive(Clone, Debug, Serialize)]
pub struct JobStates {
    pub job_id: String,
    /// `sacct` or `squeue`, whichever answered.
    pub source: String,
    /// State → number of array tasks (squeue lists only tasks not yet finished).
    pub states: BTreeMap<String, usize>,
    /// Why neither answered, when so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// A Slurm query that gave no answer.
#[derive(Debug, thiserror::Error)]
pub enum QueryError {
    #[error("{cmd}: {source}")]
    Spawn { cmd: String, source: std::io::Error },
    #[error("{cmd}: {stderr}")]
    Failed { cmd: String, stderr: String },
}

fn run(cmd: &str, args: &[&str]) -> Result<String, QueryError> {
    match Command::new(cmd).args(args).output() {
        Ok(o) if o.status.success() => Ok(String::from_utf8_lossy(&o.stdout).into_owned()),
        Ok(o) => Err(QueryError::Failed {
            cmd: cmd.into(),
            stderr: String::from_utf8_lossy(&o.stderr).trim().to_string(),
        }),
        Err(source) => Err(QueryError::Spawn {
            cmd: cmd.into(),
            source,
        }),
    }
}

/// `slurm job ID (source): STATE N, … [note]`.
impl std::fmt::Display for JobStates {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let st: Vec<String> = self
            .states
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect();
        write!(f, "slurm job {} ({}): ", self.job_id, self.source)?;
        match st.is_empty() {
            true => write!(f, "nothing queued or running")?,
            false => write!(f, "{}", st.join(", "))?,
        }
        match &self.note {
            Some(n) => write!(f, " [{n}]"),
            None => Ok(()),
        }
    }
}

/// Array-task states from `sacct`, or from `squeue` when accounting is
/// off (as on a minimal cluster).
pub fn job_states(job_id: &str) -> JobStates {
    let mut notes = Vec::new();
    match run(
        "sacct",
        &["-j", job_id, "-X", "-n", "-P", "-o", "JobID,State"],
    ) {
        Ok(text) => {
            let mut states = BTreeMap::new();
            for line in text.lines() {
                if let Some((_, st)) = line.split_once('|') {
                    let st = st.split_whitespace().next().unwrap_or("").to_string();
                    *states.entry(st).or_insert(0) += 1;
                }
            }
            return JobStates {
                job_id: job_id.into(),
                source: "sacct".into(),
                states,
                note: None,
            };
        }
        Err(e) => notes.push(e.to_string()),
    }
    match run("squeue", &["-j", job_id, "-r", "-h", "-o", "%T"]) {
        Ok(text) => {
            let mut states = BTreeMap::new();
            for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
                *states.entry(line.to_string()).or_insert(0) += 1;
            }
            JobStates {
                job_id: job_id.into(),
                source: "squeue".into(),
                states,
                note: Some(notes.join("; ")),
            }
        }
        Err(e) => {
            notes.push(e.to_string());
            JobStates {
                job_id: job_id.into(),
                source: "none".into(),
                states: BTreeMap::new(),
                note: Some(notes.join("; ")),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_has_the_array_and_options() {
        let o = SlurmOptions {
            partition: Some("short".into()),
            time: Some("00:10:00".into()),
            cpus_per_task: Some(4),
            max_parallel: Some(3),
            jobs: None,
        };
        let s = script(Path::new("/data/sw eep"), Path::new("/opt/gloam"), 12, &o).unwrap();
        assert!(s.contains("#SBATCH --array=0-11%3\n"), "{s}");
        assert!(s.contains("#SBATCH --partition=short\n"));
        assert!(s.contains("#SBATCH --time=00:10:00\n"));
        assert!(s.contains("#SBATCH --cpus-per-task=4\n"));
        assert!(s.contains(
            "exec '/opt/gloam' sweep run '/data/sw eep' --chunk \"$SLURM_ARRAY_TASK_ID\"\n"
        ));
        // --jobs reaches each array task's `sweep run`.
        let j = SlurmOptions {
            jobs: Some(7),
            ..Default::default()
        };
        let s = script(Path::new("/d"), Path::new("/g"), 1, &j).unwrap();
        assert!(
            s.contains("--chunk \"$SLURM_ARRAY_TASK_ID\" --jobs 7\n"),
            "{s}"
        );
        let bad = SlurmOptions {
            partition: Some("a\n#SBATCH --x".into()),
            ..Default::default()
        };
        assert!(script(Path::new("/d"), Path::new("/g"), 1, &bad).is_err());
        assert!(script(Path::new("/d"), Path::new("/g"), 0, &o).is_err());
    }

    #[test]
    fn time_limits_are_sbatch_forms() {
        // `man sbatch`, --time: every form it lists, and words it does not.
        for t in [
            "30",
            "0",
            "30:00",
            "01:00:00",
            "2-12",
            "2-12:30",
            "2-12:30:15",
            "UNLIMITED",
            "infinite",
        ] {
            assert!(check_time(t).is_ok(), "{t}");
        }
        for t in [
            "abc",
            "",
            "1:2:3:4",
            "1::2",
            ":30",
            "2-",
            "-12",
            "2-1:2:3:4",
            "1.5",
            "1-2-3",
            "+30",
        ] {
            assert!(check_time(t).is_err(), "{t}");
        }
    }
}
