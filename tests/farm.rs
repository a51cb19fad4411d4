//! Farm jobs: `rift farm openjd` writes a template `openjd check` accepts and `openjd run`
//! executes end to end (rings baked to caches, 2 frames x 2 sample chunks rendered, merged),
//! and `rift farm slurm` a submission script a real single-node Slurm runs (started here, as
//! root, where slurm and munge are installed; skipped with a message otherwise). Both give the
//! frames a direct render gives, to float rounding.

use crate::common;

use common::{largest_difference, python_command, rift, root, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const FRAMES: [i64; 2] = [1001, 1002];

/// The farm job's options: portal_pair (rings, so a ring-baking step), small and quick.
fn job_args<'a>(kind: &'a str, shot: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "farm",
        kind,
        shot,
        "--frames",
        "1001-1002",
        "--sample-chunks",
        "2",
        "--spp",
        "6",
        "--res",
        "64",
        "36",
        "--output",
        "frames/pp.####.exr",
        "-o",
        out,
    ]
}

fn shot() -> PathBuf {
    root().join("examples/shots/portal_pair.toml")
}

/// Renders each frame directly and checks the farm's frame against it.
fn assert_frames_equal_direct_renders(dir: &Path) {
    for frame in FRAMES {
        let direct = format!("direct.{frame}.exr");
        let f = frame.to_string();
        let shot = shot();
        let args = [
            "render",
            shot.to_str().unwrap(),
            "--frame",
            &f,
            "--spp",
            "6",
            "--res",
            "64",
            "36",
            "-o",
            &direct,
        ];
        let r = rift(dir, &args);
        assert!(r.status.success(), "{}", stderr(&r));
        let farm = dir.join(format!("frames/pp.{frame}.exr"));
        let worst = largest_difference(&dir.join(&direct), &farm);
        assert!(
            worst <= 1e-5,
            "frame {frame}: the farm's differs by {worst:e}"
        );
    }
}

fn run(program: &str, args: &[&str], dir: &Path) -> Output {
    run_command(Command::new(program), args, dir)
}

/// The OpenJD CLI of the suite's Python environment with `args` in `dir`.
fn openjd(args: &[&str], dir: &Path) -> Output {
    run_command(python_command("openjd"), args, dir)
}

fn run_command(mut command: Command, args: &[&str], dir: &Path) -> Output {
    let program = command.get_program().to_string_lossy().into_owned();
    command
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("{program}: {e}"))
}

#[test]
fn an_openjd_job_runs_end_to_end_and_equals_direct_renders() {
    let probe = python_command("openjd").arg("--version").output();
    assert!(
        probe.is_ok_and(|o| o.status.success()),
        "the OpenJD CLI is needed: tests/setup.sh installs tests/requirements.txt"
    );
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot();
    let made = rift(d, &job_args("openjd", shot.to_str().unwrap(), "job.yaml"));
    assert!(made.status.success(), "{}", stderr(&made));
    let check = openjd(&["check", "job.yaml"], d);
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );
    // The shot lies outside the template's directory, so it is passed as a job parameter,
    // as rift's message says.
    let shot_param = format!("ShotFile={}", shot.display());
    assert!(stderr(&made).contains(&shot_param), "{}", stderr(&made));
    let args = [
        "run",
        "job.yaml",
        "-p",
        &shot_param,
        "--step",
        "Merge",
        "--run-dependencies",
    ];
    let job = openjd(&args, d);
    let log = String::from_utf8_lossy(&job.stdout);
    assert!(job.status.success(), "openjd run failed:\n{log}");
    for frame in FRAMES {
        let cache = d.join(format!(
            "frames/portal_pair.farm/rings/portal_pair.{frame}.ringcache"
        ));
        assert!(
            cache.exists(),
            "the Rings step did not bake {}",
            cache.display()
        );
    }
    assert_frames_equal_direct_renders(d);
}

#[test]
fn farm_options_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let shot = shot();
    let shot = shot.to_str().unwrap();
    for (extra, expect) in [
        (&["--sample-chunks", "0"][..], "--sample-chunks"),
        (
            &["--spp", "4", "--sample-chunks", "7"][..],
            "--sample-chunks",
        ),
        (&["--res", "0", "10"][..], "--res"),
        (&["--checkpoint", "0"][..], "--checkpoint"),
        (&["--frames", "x"][..], "--frames"),
        (&["--spp", "0"][..], "--spp"),
    ] {
        for kind in ["openjd", "slurm"] {
            let mut args = vec!["farm", kind, shot, "-o", "job.out"];
            args.extend_from_slice(extra);
            let r = rift(dir.path(), &args);
            assert_eq!(r.status.code(), Some(1), "{args:?}: {}", stderr(&r));
            assert!(stderr(&r).contains(expect), "{args:?}: {}", stderr(&r));
            assert!(!dir.path().join("job.out").exists());
        }
    }
    // Open Job Description ranges cannot hold negative frames.
    let r = rift(
        dir.path(),
        &["farm", "openjd", shot, "--frames=-2-3", "-o", "job.out"],
    );
    assert_eq!(r.status.code(), Some(1), "{}", stderr(&r));
    assert!(!dir.path().join("job.out").exists());
}

#[test]
fn the_slurm_script_is_valid_shell_with_chained_arrays() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shot = shot();
    let made = rift(d, &job_args("slurm", shot.to_str().unwrap(), "submit.sh"));
    assert!(made.status.success(), "{}", stderr(&made));
    let script = std::fs::read_to_string(d.join("submit.sh")).unwrap();
    let syntax = run("bash", &["-n", "submit.sh"], d);
    assert!(syntax.status.success(), "{}", stderr(&syntax));
    for expect in [
        "--array=0-1 \\",
        "--array=0-3 --dependency=afterok:$rings",
        "--array=0-1 --dependency=afterok:$render",
        "--signal=B:TERM@120",
        "'--resume'",
    ] {
        assert!(script.contains(expect), "no {expect:?} in:\n{script}");
    }
    // Denoising goes into the merge step alone: parts are never denoised.
    let mut args = job_args("slurm", shot.to_str().unwrap(), "denoised.sh");
    args.push("--denoise");
    let made = rift(d, &args);
    assert!(made.status.success(), "{}", stderr(&made));
    let script = std::fs::read_to_string(d.join("denoised.sh")).unwrap();
    let denoising: Vec<&str> = script
        .lines()
        .filter(|l| l.contains("'--denoise'"))
        .collect();
    assert_eq!(denoising.len(), 1, "{script}");
    assert!(denoising[0].contains("'merge'"), "{script}");
}

/// A single-node Slurm cluster of the test's own, shut down when dropped.
struct Cluster {
    conf: PathBuf,
    munged_started: bool,
}

impl Cluster {
    /// Starts munge (unless running), slurmctld and slurmd; `Err` says why it cannot here.
    fn start(dir: &Path) -> Result<Self, String> {
        let is_root = run("id", &["-u"], dir).stdout.starts_with(b"0\n");
        if !is_root {
            return Err("not root".into());
        }
        for program in ["slurmctld", "slurmd", "sbatch", "munged"] {
            if !run("sh", &["-c", &format!("command -v {program}")], dir)
                .status
                .success()
            {
                return Err(format!(
                    "{program} is not installed (tests/setup.sh installs it)"
                ));
            }
        }
        let running = run("pgrep", &["-x", "munged"], dir).status.success();
        if !running {
            std::fs::create_dir_all("/run/munge").map_err(|e| e.to_string())?;
            let m = run("munged", &["--force"], dir);
            if !m.status.success() {
                return Err(format!("munged did not start: {}", stderr(&m)));
            }
        }
        let host = String::from_utf8_lossy(&run("hostname", &["-s"], dir).stdout)
            .trim()
            .to_owned();
        let ports: Vec<u16> = (0..2)
            .map(|_| {
                let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
                l.local_addr().unwrap().port()
            })
            .collect();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let s = dir.display();
        for sub in ["state", "spool"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let conf = dir.join("slurm.conf");
        std::fs::write(
            &conf,
            format!(
                "ClusterName=rifttest\nSlurmctldHost={host}(127.0.0.1)\nAuthType=auth/munge\n\
                 ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
                 SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
                 SlurmctldPidFile={s}/slurmctld.pid\nSlurmdPidFile={s}/slurmd.pid\n\
                 SlurmdSpoolDir={s}/spool\nStateSaveLocation={s}/state\n\
                 SlurmctldLogFile={s}/slurmctld.log\nSlurmdLogFile={s}/slurmd.log\n\
                 SlurmUser=root\nSlurmctldPort={}\nSlurmdPort={}\nReturnToService=2\n\
                 MpiDefault=none\nJobCompType=jobcomp/none\n\
                 AccountingStorageType=accounting_storage/none\nSchedulerType=sched/backfill\n\
                 NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory=1000 State=UNKNOWN\n\
                 PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
                ports[0], ports[1]
            ),
        )
        .unwrap();
        let cluster = Cluster {
            conf,
            munged_started: !running,
        };
        for daemon in ["slurmctld", "slurmd"] {
            let out = cluster.command(daemon, &["-f", &cluster.conf.to_string_lossy()], dir);
            if !out.status.success() {
                return Err(format!("{daemon} did not start: {}", stderr(&out)));
            }
        }
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            let state = cluster.command("sinfo", &["-h", "-o", "%t"], dir);
            if String::from_utf8_lossy(&state.stdout).trim() == "idle" {
                return Ok(cluster);
            }
            std::thread::sleep(Duration::from_millis(500));
        }
        Err("the node never became idle".into())
    }

    fn command(&self, program: &str, args: &[&str], dir: &Path) -> Output {
        Command::new(program)
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .current_dir(dir)
            .output()
            .unwrap()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let dir = self.conf.parent().unwrap().to_owned();
        self.command("scontrol", &["shutdown"], &dir);
        if self.munged_started {
            let _ = Command::new("pkill").args(["-x", "munged"]).status();
        }
    }
}

#[test]
fn a_slurm_job_runs_on_a_real_cluster_and_equals_direct_renders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let slurm_dir = d.join("slurm");
    std::fs::create_dir(&slurm_dir).unwrap();
    let cluster = match Cluster::start(&slurm_dir) {
        Ok(c) => c,
        Err(why) => {
            eprintln!("skipped: a single-node Slurm cannot be started here: {why}");
            return;
        }
    };
    let shot = shot();
    let made = rift(d, &job_args("slurm", shot.to_str().unwrap(), "submit.sh"));
    assert!(made.status.success(), "{}", stderr(&made));
    let submitted = cluster.command("./submit.sh", &[], d);
    assert!(submitted.status.success(), "{}", stderr(&submitted));
    let deadline = Instant::now() + Duration::from_secs(240);
    let done = |f: i64| d.join(format!("frames/pp.{f}.exr")).exists();
    while !FRAMES.iter().all(|&f| done(f)) {
        let queue = cluster.command("squeue", &["-h"], d);
        let queued = String::from_utf8_lossy(&queue.stdout).trim().to_owned();
        assert!(
            Instant::now() < deadline,
            "the Slurm job did not finish in 240 s; queue:\n{queued}"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    // The merge writes atomically, so a frame that exists is whole.
    assert_frames_equal_direct_renders(d);
    drop(cluster);
}
