//! The distributed-rendering examples of docs/distributed.md, run locally on a tiny image:
//! the Slurm job-array script with a stand-in `sbatch` that runs jobs at once, and the shell
//! scripts of the Kubernetes Indexed Job manifest with JOB_COMPLETION_INDEX set by hand.
//! Both must end in a merged checkpoint equal to the sum of the per-seed checkpoints.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::Command;

use render::checkpoint::Checkpoint;
use render::image_io::read_image;

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("lucent-dist-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A folder holding `lucent` (a link to the binary under test) and, if given, more scripts.
fn bin_dir(scratch: &Path, extra: &[(&str, &str)]) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let bin = scratch.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_lucent"), bin.join("lucent")).unwrap();
    for (name, text) in extra {
        let p = bin.join(name);
        std::fs::write(&p, text).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    bin
}

fn path_with(bin: &Path) -> String {
    format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default())
}

/// The merged checkpoint must hold every seed once and equal the sum of the per-seed ones.
fn check_merged(run_dir: &Path, seeds: &[u64], spp_each: u64) {
    let merged = Checkpoint::read(&run_dir.join("merged.ckpt")).unwrap();
    let mut got: Vec<u64> = merged.runs.iter().map(|r| r.seed).collect();
    got.sort();
    assert_eq!(got, seeds);
    assert_eq!(merged.film.samples_per_pixel(), spp_each * seeds.len() as u64);
    let mut sum = Checkpoint::read(&run_dir.join(format!("seed-{}.ckpt", seeds[0]))).unwrap().film;
    for s in &seeds[1..] {
        sum.add_film(&Checkpoint::read(&run_dir.join(format!("seed-{s}.ckpt"))).unwrap().film).unwrap();
    }
    for (a, b) in merged.film.sums().iter().zip(sum.sums()) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() <= 1e-12 * b[k].abs().max(1.0), "merged sums differ: {a:?} vs {b:?}");
        }
    }
    assert_eq!(read_image(&run_dir.join("merged.exr")).unwrap(), merged.film.to_image());
    assert!(run_dir.join("merged.png").exists());
}

/// Stand-in for Slurm's `sbatch`: runs the script at once (array tasks one after another) with
/// the variables Slurm would set, and prints a job id as `--parsable` does.
const FAKE_SBATCH: &str = r#"#!/usr/bin/env bash
set -euo pipefail
array=""; chdir="."; script=""
for a in "$@"; do
  case "$a" in
    --array=*) array=${a#--array=} ;;
    --chdir=*) chdir=${a#--chdir=} ;;
    --*) ;;
    *) script=$(cd "$(dirname "$a")" && pwd)/$(basename "$a") ;;
  esac
done
cd "$chdir"
if [[ -n "$array" ]]; then
  for ((i = ${array%-*}; i <= ${array#*-}; i++)); do
    SLURM_ARRAY_TASK_ID=$i SLURM_CPUS_PER_TASK=1 bash "$script" >>fake-slurm.log 2>&1
  done
else
  bash "$script" >>fake-slurm.log 2>&1
fi
echo $((RANDOM + 1000))
"#;

#[test]
fn slurm_job_array_script_renders_each_seed_and_merges() {
    let t = Scratch::new("slurm");
    let bin = bin_dir(&t.0, &[("sbatch", FAKE_SBATCH)]);
    let run_dir = t.0.join("run");
    let submit = |offset: &str| {
        let out = Command::new("bash")
            .arg(format!("{REPO}/examples/slurm/render-array.sh"))
            .args(["builtin", "3", "4"])
            .current_dir(&t.0)
            .env("PATH", path_with(&bin))
            .env("RUN_DIR", &run_dir)
            .env("SEED_OFFSET", offset)
            .env("EXTRA_ARGS", "--width 16 --height 12")
            .env_remove("LUCENT")
            .output()
            .unwrap();
        let log = std::fs::read_to_string(run_dir.join("fake-slurm.log")).unwrap_or_default();
        assert!(out.status.success(), "{}\n{}\n{log}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    };
    submit("0");
    check_merged(&run_dir, &[0, 1, 2], 4);
    // Resubmitting the same run resumes each finished task (no new samples) and merges again.
    submit("0");
    check_merged(&run_dir, &[0, 1, 2], 4);
    // More seeds later: a second array with SEED_OFFSET=3 adds seeds 3..5 to the merge.
    submit("3");
    check_merged(&run_dir, &[0, 1, 2, 3, 4, 5], 4);
}

/// The block scalar after the `marker` line's `args:` in the manifest, dedented.
fn script_after(manifest: &str, marker: &str) -> String {
    let start = manifest.find(marker).unwrap_or_else(|| panic!("{marker} not in manifest"));
    let rest = &manifest[start..];
    let block = rest.find("- |\n").expect("no block scalar after marker");
    let line_start = rest[..block].rfind('\n').map_or(0, |i| i + 1);
    let mut lines = rest[line_start..].lines();
    let head = lines.next().unwrap();
    let indent = head.len() - head.trim_start().len();
    let mut script = String::new();
    for l in lines {
        let l_indent = l.len() - l.trim_start().len();
        if !l.trim().is_empty() && l_indent <= indent {
            break;
        }
        script.push_str(l.get(indent + 2..).unwrap_or(""));
        script.push('\n');
    }
    script
}

#[test]
fn kubernetes_indexed_job_scripts_render_each_index_and_merge() {
    let t = Scratch::new("k8s");
    let bin = bin_dir(&t.0, &[]);
    let manifest = std::fs::read_to_string(format!("{REPO}/examples/k8s/render-indexed-job.yaml")).unwrap();
    let render = script_after(&manifest, "name: lucent-render");
    let wait = script_after(&manifest, "name: wait-for-renders");
    let merge = script_after(&manifest, "- name: merge");
    let run_dir = t.0.join("data/run");
    let sh = |script: &str, envs: &[(&str, String)]| {
        let mut c = Command::new("sh");
        c.args(["-c", script]).current_dir(&t.0).env("PATH", path_with(&bin)).env("RUN", &run_dir);
        for (k, v) in envs {
            c.env(k, v);
        }
        let out = c.output().unwrap();
        assert!(out.status.success(), "script failed:\n{script}\n{}", String::from_utf8_lossy(&out.stderr));
    };
    for index in 0..3 {
        sh(&render, &[
            ("JOB_COMPLETION_INDEX", index.to_string()),
            ("SCENE", "builtin".into()),
            ("SPP", "4".into()),
            ("THREADS", "1".into()),
            ("EXTRA_ARGS", "--width 16 --height 12".into()),
        ]);
    }
    // A retried pod of index 1 resumes its finished checkpoint: no extra samples.
    sh(&render, &[
        ("JOB_COMPLETION_INDEX", "1".into()),
        ("SCENE", "builtin".into()),
        ("SPP", "4".into()),
        ("THREADS", "1".into()),
        ("EXTRA_ARGS", "--width 16 --height 12".into()),
    ]);
    sh(&wait, &[("TASKS", "3".into())]);
    sh(&merge, &[]);
    check_merged(&run_dir, &[0, 1, 2], 4);
}

/// Slurm's `--signal=B:INT@120` interrupts the batch script before the time limit: the script
/// must pass SIGINT on to lucent, which saves its checkpoint and image and exits 130.
#[test]
fn slurm_task_passes_sigint_on_so_lucent_saves_and_exits_130() {
    use std::time::{Duration, Instant};
    let t = Scratch::new("slurm-signal");
    let bin = bin_dir(&t.0, &[]);
    let run_dir = t.0.join("run");
    std::fs::create_dir_all(&run_dir).unwrap();
    let mut task = Command::new("bash");
    task.arg(format!("{REPO}/examples/slurm/render-array.sh"))
        .current_dir(&run_dir)
        .env("PATH", path_with(&bin))
        .env("LUCENT_PHASE", "render")
        .env("SCENE", "builtin")
        .env("SPP", "100000000")
        .env("RUN_DIR", &run_dir)
        .env("SEED_OFFSET", "10")
        .env("SLURM_ARRAY_TASK_ID", "2")
        .env("SLURM_CPUS_PER_TASK", "1")
        .env("EXTRA_ARGS", "--width 16 --height 12 --checkpoint-interval 0.05")
        .env_remove("LUCENT")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null());
    // Slurm starts the batch script with SIGINT at its default action. A test run started in the
    // background of a non-interactive shell (`nohup cargo test &`) inherits SIGINT ignored, and a
    // shell cannot trap a signal ignored on entry (POSIX), so give the script Slurm's disposition.
    // SAFETY: `signal` is async-signal-safe, as `pre_exec` requires.
    unsafe {
        use std::os::unix::process::CommandExt;
        task.pre_exec(|| {
            libc::signal(libc::SIGINT, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut task = task.spawn().unwrap();
    let ckpt = run_dir.join("seed-12.ckpt");
    let deadline = Instant::now() + Duration::from_secs(120);
    while !ckpt.exists() {
        assert!(Instant::now() < deadline, "no checkpoint within 120 s");
        assert!(task.try_wait().unwrap().is_none(), "task ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(100));
    assert!(Command::new("kill").args(["-INT", &task.id().to_string()]).status().unwrap().success());
    // The stop gets its own minute, however long the first checkpoint took on a loaded machine.
    let stop_deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = task.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > stop_deadline {
            let _ = task.kill();
            panic!("task did not stop within 60 s of SIGINT (lucent left running?)");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(130));
    let ck = Checkpoint::read(&ckpt).unwrap();
    assert_eq!(ck.resume_point(&ckpt).unwrap().0, 12);
    assert_eq!(read_image(&run_dir.join("seed-12.exr")).unwrap(), ck.film.to_image());
}

/// Kubernetes stops a pod with SIGTERM: the render container's script turns it into SIGINT,
/// lucent saves and exits 130, and the pod is not marked done (so the merge keeps waiting).
#[test]
fn kubernetes_render_script_turns_sigterm_into_a_saved_checkpoint() {
    use std::time::{Duration, Instant};
    let t = Scratch::new("k8s-signal");
    let bin = bin_dir(&t.0, &[]);
    let manifest = std::fs::read_to_string(format!("{REPO}/examples/k8s/render-indexed-job.yaml")).unwrap();
    let render = script_after(&manifest, "name: lucent-render");
    let run_dir = t.0.join("data/run");
    let mut pod = Command::new("sh")
        .args(["-c", &render])
        .current_dir(&t.0)
        .env("PATH", path_with(&bin))
        .env("RUN", &run_dir)
        .env("JOB_COMPLETION_INDEX", "5")
        .env("SCENE", "builtin")
        .env("SPP", "100000000")
        .env("THREADS", "1")
        .env("EXTRA_ARGS", "--width 16 --height 12 --checkpoint-interval 0.05")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let ckpt = run_dir.join("seed-5.ckpt");
    let deadline = Instant::now() + Duration::from_secs(120);
    while !ckpt.exists() {
        assert!(Instant::now() < deadline, "no checkpoint within 120 s");
        assert!(pod.try_wait().unwrap().is_none(), "pod script ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(100));
    assert!(Command::new("kill").args(["-TERM", &pod.id().to_string()]).status().unwrap().success());
    let stop_deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = pod.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > stop_deadline {
            let _ = pod.kill();
            panic!("pod script did not stop within 60 s of SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(130));
    assert!(!run_dir.join("seed-5.done").exists());
    let ck = Checkpoint::read(&ckpt).unwrap();
    assert_eq!(ck.resume_point(&ckpt).unwrap().0, 5);
    assert!(ck.film.samples_per_pixel() >= 1);
}
