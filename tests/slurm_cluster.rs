//! A real one-node Slurm cluster (munged, slurmctld, slurmd in a temp
//! directory on private ports) runs the 12-task sweep and a 4-tile render
//! as array jobs; the results must be identical to the local run's.
//!
//! Needs Debian's `slurm-wlm` and `munge` and root (`.ci/run` installs
//! them). Without them the test says so loudly; with
//! `GLOAM_REQUIRE_SLURM=1` (as in CI) it fails instead of passing.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn gloam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gloam"))
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn which(cmd: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/sbin")])
        .map(|d| d.join(cmd))
        .find(|p| p.is_file())
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// The daemons this test started, stopped by the PIDs in their pid files.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
}

impl Cluster {
    fn pid_files(&self) -> [PathBuf; 3] {
        let d = self.dir.path();
        [
            d.join("slurmd.pid"),
            d.join("slurmctld.pid"),
            d.join("munged.pid"),
        ]
    }

    fn logs(&self) -> String {
        let mut s = String::new();
        for f in ["slurmctld.log", "slurmd.log", "munged.log"] {
            let text = std::fs::read_to_string(self.dir.path().join(f)).unwrap_or_default();
            let tail: Vec<&str> = text.lines().rev().take(25).collect();
            s.push_str(&format!("--- {f} (last lines)\n"));
            for l in tail.iter().rev() {
                s.push_str(l);
                s.push('\n');
            }
        }
        s
    }

    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    fn start() -> Result<Cluster, String> {
        let dir = tempfile::Builder::new()
            .prefix("gloam-slurm-")
            .tempdir()
            .map_err(|e| e.to_string())?;
        let d = dir.path().to_path_buf();
        // munged wants its socket's directory reachable by everyone.
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o755))
            .map_err(|e| e.to_string())?;
        let key: Vec<u8> = {
            let mut k = vec![0u8; 1024];
            use std::io::Read;
            std::fs::File::open("/dev/urandom")
                .and_then(|mut f| f.read_exact(&mut k))
                .map_err(|e| e.to_string())?;
            k
        };
        let key_file = d.join("munge.key");
        std::fs::write(&key_file, key).map_err(|e| e.to_string())?;
        std::fs::set_permissions(&key_file, std::fs::Permissions::from_mode(0o400))
            .map_err(|e| e.to_string())?;
        for sub in ["state", "spool"] {
            std::fs::create_dir(d.join(sub)).map_err(|e| e.to_string())?;
        }
        let host = String::from_utf8(
            Command::new("hostname")
                .arg("-s")
                .output()
                .map_err(|e| e.to_string())?
                .stdout,
        )
        .map_err(|e| e.to_string())?
        .trim()
        .to_string();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let p = |f: &str| d.join(f).display().to_string();
        let conf = d.join("slurm.conf");
        let text = format!(
            "ClusterName=gloamtest\n\
             SlurmctldHost={host}(127.0.0.1)\n\
             SlurmctldPort={}\n\
             SlurmdPort={}\n\
             AuthType=auth/munge\n\
             AuthInfo=socket={}\n\
             CredType=cred/munge\n\
             ProctrackType=proctrack/linuxproc\n\
             TaskPlugin=task/none\n\
             JobAcctGatherType=jobacct_gather/none\n\
             SelectType=select/cons_tres\n\
             SlurmUser=root\n\
             SlurmdUser=root\n\
             StateSaveLocation={}\n\
             SlurmdSpoolDir={}\n\
             SlurmctldPidFile={}\n\
             SlurmdPidFile={}\n\
             SlurmctldLogFile={}\n\
             SlurmdLogFile={}\n\
             ReturnToService=2\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
             PartitionName=gloam Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            free_port(),
            free_port(),
            p("munge.sock"),
            p("state"),
            p("spool"),
            p("slurmctld.pid"),
            p("slurmd.pid"),
            p("slurmctld.log"),
            p("slurmd.log"),
        );
        std::fs::write(&conf, text).map_err(|e| e.to_string())?;
        let cluster = Cluster { dir, conf };
        let run = |c: &mut Command, what: &str| -> Result<(), String> {
            let o = c.output().map_err(|e| format!("{what}: {e}"))?;
            if o.status.success() {
                Ok(())
            } else {
                Err(format!(
                    "{what} failed: {}",
                    String::from_utf8_lossy(&o.stderr)
                ))
            }
        };
        let bin = |c: &str| which(c).unwrap_or_else(|| PathBuf::from(c));
        run(
            Command::new(bin("munged"))
                .arg(format!("--key-file={}", p("munge.key")))
                .arg(format!("--socket={}", p("munge.sock")))
                .arg(format!("--pid-file={}", p("munged.pid")))
                .arg(format!("--log-file={}", p("munged.log")))
                .arg(format!("--seed-file={}", p("munge.seed"))),
            "munged",
        )?;
        run(
            Command::new(bin("slurmctld")).arg("-f").arg(&cluster.conf),
            "slurmctld",
        )?;
        run(
            Command::new(bin("slurmd")).arg("-f").arg(&cluster.conf),
            "slurmd",
        )?;
        // Idle within a bounded time.
        let t0 = Instant::now();
        loop {
            let o = cluster.cmd("sinfo").args(["-h", "-o", "%T"]).output();
            if let Ok(o) = o {
                if String::from_utf8_lossy(&o.stdout).trim() == "idle" {
                    break;
                }
            }
            if t0.elapsed() > Duration::from_secs(60) {
                return Err(format!(
                    "the node did not become idle in 60 s\n{}",
                    cluster.logs()
                ));
            }
            std::thread::sleep(Duration::from_millis(250));
        }
        Ok(cluster)
    }

    /// Waits until `gloam sweep status DIR` reports every task done.
    fn wait_for(&self, dir: &Path, total: u64, timeout: Duration) {
        let t0 = Instant::now();
        loop {
            let o = gloam()
                .env("SLURM_CONF", &self.conf)
                .args(["sweep", "status"])
                .arg(dir)
                .arg("--json")
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let failed = v["tasks"]["failed"].as_array().map_or(0, Vec::len);
            assert_eq!(failed, 0, "tasks failed on Slurm: {v:#}\n{}", self.logs());
            if v["tasks"]["done"].as_u64() == Some(total) {
                return;
            }
            assert!(
                t0.elapsed() < timeout,
                "Slurm did not finish {total} tasks in {timeout:?}: {v:#}\n{}\njob output: {}",
                self.logs(),
                job_outputs(dir)
            );
            std::thread::sleep(Duration::from_millis(500));
        }
    }
}

fn job_outputs(dir: &Path) -> String {
    let mut s = String::new();
    if let Ok(rd) = std::fs::read_dir(dir.join("slurm")) {
        for e in rd.flatten() {
            s.push_str(&format!(
                "\n{}: {}",
                e.path().display(),
                std::fs::read_to_string(e.path()).unwrap_or_default()
            ));
        }
    }
    s
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for f in self.pid_files() {
            if let Ok(pid) = std::fs::read_to_string(&f) {
                let pid = pid.trim();
                if !pid.is_empty() && pid.chars().all(|c| c.is_ascii_digit()) {
                    let _ = Command::new("kill").arg(pid).status();
                }
            }
        }
        // Let them exit before their directory goes.
        std::thread::sleep(Duration::from_millis(500));
    }
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run");
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Straight to stderr: the test harness captures `eprintln!` of a passing
/// test, and this notice must be seen.
fn loud(msg: &str) {
    use std::io::Write;
    let bar = "!".repeat(msg.len().min(100));
    let _ = writeln!(std::io::stderr(), "\n{bar}\n{msg}\n{bar}\n");
}

#[test]
fn a_real_slurm_runs_the_sweep_and_a_tiled_render_like_the_local_run() {
    let missing: Vec<&str> = ["munged", "slurmctld", "slurmd", "sbatch", "sinfo"]
        .into_iter()
        .filter(|c| which(c).is_none())
        .collect();
    if !missing.is_empty() {
        let msg = format!(
            "SLURM TEST NOT RUN: {} not installed (apt-get install slurm-wlm munge; .ci/run does)",
            missing.join(", ")
        );
        loud(&msg);
        assert!(
            std::env::var("GLOAM_REQUIRE_SLURM").as_deref() != Ok("1"),
            "{msg}, and GLOAM_REQUIRE_SLURM=1"
        );
        return;
    }
    let cluster = match Cluster::start() {
        Ok(c) => c,
        Err(e) => {
            let msg = format!("SLURM TEST NOT RUN: the one-node cluster did not start: {e}");
            loud(&msg);
            assert!(
                std::env::var("GLOAM_REQUIRE_SLURM").as_deref() != Ok("1"),
                "{msg}"
            );
            return;
        }
    };
    let tmp = tempfile::tempdir().unwrap();
    let twelve = root().join("tests/sweep/twelve.toml");
    let tiles = root().join("tests/sweep/tiles4.toml");

    // Submit both before waiting, so they share the node.
    let on_slurm = tmp.path().join("slurm-twelve");
    let tiled = tmp.path().join("slurm-tiles");
    for (sweep, dir) in [(&twelve, &on_slurm), (&tiles, &tiled)] {
        let id = run_ok(
            gloam()
                .env("SLURM_CONF", &cluster.conf)
                .arg("sweep")
                .arg(sweep)
                .arg("--out")
                .arg(dir)
                .args([
                    "--slurm",
                    "--partition",
                    "gloam",
                    "--time",
                    "10",
                    "--cpus-per-task",
                    "1",
                    "--max-parallel",
                    "4",
                ]),
        );
        assert!(
            id.trim().chars().all(|c| c.is_ascii_digit()),
            "job id: {id}"
        );
        let script = std::fs::read_to_string(dir.join("sweep.sbatch")).unwrap();
        assert!(
            script.contains("%4\n") && script.contains("--partition=gloam"),
            "{script}"
        );
    }

    // Meanwhile, the same work locally.
    let local = tmp.path().join("local-twelve");
    let out = gloam()
        .arg("sweep")
        .arg(&twelve)
        .arg("--out")
        .arg(&local)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let whole = tmp.path().join("whole");
    let one = tmp.path().join("one.toml");
    std::fs::write(
        &one,
        std::fs::read_to_string(&tiles)
            .unwrap()
            .replace("../../sims", &root().join("sims").display().to_string())
            .replace("tile = [\"1/4\", \"2/4\", \"3/4\", \"4/4\"]", "seed = [0]"),
    )
    .unwrap();
    let out = gloam()
        .arg("sweep")
        .arg(&one)
        .arg("--out")
        .arg(&whole)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    cluster.wait_for(&on_slurm, 12, Duration::from_secs(300));
    cluster.wait_for(&tiled, 4, Duration::from_secs(300));

    // Slurm's view of the job, through `gloam sweep status`.
    let st = run_ok(
        gloam()
            .env("SLURM_CONF", &cluster.conf)
            .args(["sweep", "status"])
            .arg(&on_slurm),
    );
    assert!(
        st.contains("12 task(s): 12 done") && st.contains("slurm job"),
        "{st}"
    );

    run_ok(gloam().args(["sweep", "collect"]).arg(&on_slurm));
    for f in ["results.csv", "results.json"] {
        let a = std::fs::read(local.join(f)).unwrap();
        let b = std::fs::read(on_slurm.join(f)).unwrap();
        assert!(a == b, "{f} from Slurm differs from the local run's");
    }
    let dirs: Vec<PathBuf> = (0..4)
        .map(|i| tiled.join(format!("tasks/{i:05}")))
        .collect();
    let merged = tmp.path().join("merged");
    run_ok(gloam().arg("merge").args(&dirs).arg("--out").arg(&merged));
    for f in [
        "radiance.npy",
        "stderr.npy",
        "spp.npy",
        "radiance.tiff",
        "preview.png",
    ] {
        let a = std::fs::read(whole.join("tasks/00000").join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(
            a == b,
            "{f} merged from Slurm tiles differs from the local untiled render"
        );
    }
    drop(cluster);
}
